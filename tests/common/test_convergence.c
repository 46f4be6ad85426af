/* The convergence log and the no-reference error estimate: the log's text form, its trip
 * through a film file and through merging, and the estimate checked against the true error
 * of a real render measured against a much longer, independent reference. */
#define _GNU_SOURCE /* memmem */
#include "check.h"
#include "film_fixtures.h"
#include "common/convergence.h"
#include "common/error.h"
#include "common/film.h"
#include "worker/render/render.h"
#include "worker/scene/load.h"

#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

static vf_convergence_entry entry(uint32_t run, double wall, uint64_t iterations, double rmse, double estimate) {
  vf_convergence_entry e = {run, wall, 2 * wall, iterations, rmse, isnan(rmse) ? NAN : rmse * 3, estimate};
  return e;
}

static int same_double(double a, double b) { return (isnan(a) && isnan(b)) || fabs(a - b) <= 1e-8 * fabs(a); }

static int entries_equal(const vf_convergence_entry *a, const vf_convergence_entry *b) {
  return a->run == b->run && a->iterations == b->iterations && same_double(a->wall_seconds, b->wall_seconds) &&
         same_double(a->cpu_seconds, b->cpu_seconds) && same_double(a->rmse, b->rmse) &&
         same_double(a->rel_mse, b->rel_mse) && same_double(a->estimated_rmse, b->estimated_rmse);
}

static void test_log_text_round_trips(void) {
  vf_convergence_log log, back;
  vf_convergence_init(&log);
  vf_convergence_init(&back);
  vf_convergence_entry e[3] = {entry(0, 10.5, 16, NAN, 0.25), entry(0, 20.25, 33, 0.125, 0.1171875),
                               entry(2, 1e-3, 1ULL << 40, 1e-30, NAN)};
  for (int i = 0; i < 3; i++) CHECK_INT_EQ(vf_convergence_append(&log, &e[i]), VF_OK);
  char *text = NULL;
  CHECK_INT_EQ(vf_convergence_format(&log, &text), VF_OK);
  printf("  text:\n%s", text);
  CHECK_INT_EQ(vf_convergence_parse(&back, text, "x.exr"), VF_OK);
  CHECK_INT_EQ(back.count, 3);
  for (size_t i = 0; i < back.count && i < 3; i++) CHECK(entries_equal(&back.entries[i], &e[i]));
  free(text);
  vf_convergence_destroy(&back);
  CHECK_INT_EQ(vf_convergence_parse(&back, "", "x.exr"), VF_OK); /* the empty log */
  CHECK_INT_EQ(back.count, 0);
  vf_convergence_destroy(&log);
}

static void test_malformed_log_text_is_refused(void) {
  static const char *const bad[] = {
      "0 1 2 3 nan nan 0.5",             /* no newline */
      "0 1 2 3 nan nan\n",               /* six fields */
      "0  1 2 3 nan nan 0.5\n",          /* two blanks */
      "-1 1 2 3 nan nan 0.5\n",          /* negative run */
      "0 -1 2 3 nan nan 0.5\n",          /* negative time */
      "0 inf 2 3 nan nan 0.5\n",         /* infinite time */
      "0 1 2 3 -0.5 nan 0.5\n",          /* negative error */
      "0 1 2 3 nan nan inf\n",           /* infinite estimate */
      "0 1 2 3.5 nan nan 0.5\n",         /* fractional iterations */
      "1 1 2 3 nan nan 0.5\n0 2 3 4 nan nan 0.4\n", /* runs decrease */
      "0 1 2 3 nan nan 0.5\ngarbage\n",
  };
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    vf_convergence_log log;
    vf_convergence_init(&log);
    int err = vf_convergence_parse(&log, bad[i], "f.exr");
    CHECK_INT_EQ(err, VF_EFILM);
    if (err == VF_EFILM) CHECK_STR_CONTAINS(vf_error_detail(err), "f.exr: attribute vcmfarm:convergence: entry");
    CHECK_INT_EQ(log.count, 0);
  }
}

/* A film whose iterations are a fixed function of their index, as in test_film, of the
 * settings `settings` ("algorithm=vcm resolution=WxH" when NULL). */
static vf_film *synthetic_film_of(int w, int h, uint64_t begin, uint64_t end, const char *settings) {
  vf_film *film = NULL;
  if (vf_film_create(w, h, &film) != VF_OK) return NULL;
  if (settings) snprintf(film->settings_text, sizeof film->settings_text, "%s", settings);
  float *cam = malloc(sizeof(float) * 3 * (size_t)(w * h)), *light = malloc(sizeof(float) * 3 * (size_t)(w * h));
  for (uint64_t k = begin; k < end; k++) {
    for (int i = 0; i < 3 * w * h; i++) {
      cam[i] = (float)((k * 7 + (uint64_t)i * 13) % 10) * 0.1f;
      light[i] = (k % 2) ? 0.05f : 0.0f;
    }
    vf_film_add_iteration(film, k, cam, light, NULL);
  }
  free(cam);
  free(light);
  memset(film->scene_hash, 0x5a, sizeof film->scene_hash);
  if (!settings) snprintf(film->settings_text, sizeof film->settings_text, "algorithm=vcm resolution=%dx%d", w, h);
  film->render_seconds = 0.5 * (double)(end - begin);
  film->cpu_seconds = 0.9 * (double)(end - begin);
  return film;
}

static vf_film *synthetic_film(int w, int h, uint64_t begin, uint64_t end) {
  return synthetic_film_of(w, h, begin, end, NULL);
}

/* A sobol film's estimate is the spread of its two replicates' means (even and odd
 * iterations, common/film.c), whatever the split of its iterations between films. */
#define SOBOL_SETTINGS "algorithm=pt max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3 sampler=sobol"
static void test_sobol_estimate_is_the_spread_of_the_replicates(void) {
  vf_film *f = synthetic_film_of(4, 3, 0, 7, SOBOL_SETTINGS);
  if (!f) return;
  CHECK(vf_film_sobol(f));
  double total = 0.0;
  for (int i = 0; i < 3 * 4 * 3; i++) {
    double s[2] = {0, 0}, n[2] = {0, 0};
    for (int k = 0; k < 7; k++) {
      double x = (double)(float)((float)((k * 7 + i * 13) % 10) * 0.1f) + ((k % 2) ? (double)0.05f : 0.0);
      s[k % 2] += x;
      n[k % 2] += 1;
    }
    double m = (s[0] + s[1]) / 7, m0 = s[0] / n[0], m1 = s[1] / n[1];
    total += (n[0] * (m0 - m) * (m0 - m) + n[1] * (m1 - m) * (m1 - m)) / 7;
  }
  CHECK_NEAR(vf_film_estimate_rmse(f), sqrt(total / 36), 1e-12);
  vf_film *a = synthetic_film_of(4, 3, 0, 3, SOBOL_SETTINGS), *b = synthetic_film_of(4, 3, 3, 7, SOBOL_SETTINGS);
  CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
  CHECK_NEAR(vf_film_estimate_rmse(a), vf_film_estimate_rmse(f), 1e-12);
  vf_film *even = synthetic_film_of(4, 3, 2, 3, SOBOL_SETTINGS); /* one replicate alone: no estimate */
  CHECK(isnan(vf_film_estimate_rmse(even)));
  vf_film_destroy(even);
  vf_film_destroy(a);
  vf_film_destroy(b);
  vf_film_destroy(f);
}

static void test_estimate_is_the_standard_error_of_the_mean(void) {
  vf_film *f = synthetic_film(4, 3, 0, 7);
  if (!f) return;
  /* the same formula, written out per value from the per-iteration estimates as the film
   * holds them (docs/FILM.md, "Exact sums": x to the nearest 2^-32, x^2 to the nearest
   * 2^-16), and beside it from the raw estimates, which the rounding of the squares moves
   * by less than a millionth */
  double total = 0.0, raw_total = 0.0;
  for (int i = 0; i < 3 * 4 * 3; i++) {
    double x[7], m = 0.0, s2 = 0.0, held_sum = 0.0, held_squares = 0.0;
    for (int k = 0; k < 7; k++) {
      x[k] = (double)(float)((float)((k * 7 + i * 13) % 10) * 0.1f) + ((k % 2) ? (double)0.05f : 0.0);
      m += x[k] / 7;
      held_sum += nearbyint(x[k] * 0x1p32) * 0x1p-32;
      held_squares += nearbyint(x[k] * x[k] * 0x1p16) * 0x1p-16;
    }
    for (int k = 0; k < 7; k++) s2 += (x[k] - m) * (x[k] - m) / 6;
    raw_total += s2 / 7;
    double held_mean = held_sum / 7;
    total += (held_squares - 7 * held_mean * held_mean) / 6 / 7;
  }
  CHECK_NEAR(vf_film_estimate_rmse(f), sqrt(total / 36), 1e-12);
  CHECK_NEAR(vf_film_estimate_rmse(f), sqrt(raw_total / 36), 1e-6 * sqrt(raw_total / 36));
  vf_film *one = synthetic_film(4, 3, 0, 1);
  CHECK(isnan(vf_film_estimate_rmse(one)));
  /* it uses sums only: the merge of two halves has the estimate of the whole */
  vf_film *a = synthetic_film(4, 3, 0, 3), *b = synthetic_film(4, 3, 3, 7);
  CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
  CHECK_NEAR(vf_film_estimate_rmse(a), vf_film_estimate_rmse(f), 1e-12);
  vf_film_destroy(a);
  vf_film_destroy(b);
  vf_film_destroy(one);
  vf_film_destroy(f);
}

static void test_merge_appends_the_source_log_as_new_runs(void) {
  vf_film *a = synthetic_film(4, 3, 0, 3), *b = synthetic_film(4, 3, 3, 7), *c = synthetic_film(4, 3, 2, 4);
  if (!a || !b || !c) return;
  vf_convergence_entry ea[2] = {entry(0, 1, 2, NAN, 0.5), entry(1, 1.5, 3, NAN, 0.4)};
  vf_convergence_entry eb[2] = {entry(3, 1, 2, 0.6, 0.5), entry(3, 2, 4, 0.4, 0.4)};
  for (int i = 0; i < 2; i++) {
    vf_convergence_append(&a->convergence, &ea[i]);
    vf_convergence_append(&b->convergence, &eb[i]);
  }
  snprintf(b->scene_name, sizeof b->scene_name, "cornell");
  CHECK_INT_EQ(vf_film_merge(a, c), VF_EOVERLAP); /* refused: log unchanged */
  CHECK_INT_EQ(a->convergence.count, 2);
  CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
  CHECK_INT_EQ(a->convergence.count, 4);
  if (a->convergence.count == 4) {
    CHECK_INT_EQ(a->convergence.entries[1].run, 1);
    CHECK_INT_EQ(a->convergence.entries[2].run, 2); /* b's run 3 follows a's last run */
    CHECK_INT_EQ(a->convergence.entries[3].run, 2);
    CHECK_NEAR(a->convergence.entries[3].rmse, 0.4, 0);
  }
  CHECK(strcmp(a->scene_name, "cornell") == 0);
  CHECK_NEAR(a->cpu_seconds, 0.9 * 7, 1e-12);
  CHECK_INT_EQ(vf_convergence_validate(&a->convergence, "a"), VF_OK);
  /* a new session continues run 2 only while the film is the one it measured */
  CHECK_INT_EQ(vf_convergence_next_run(&a->convergence, 7, a->render_seconds), 3);
  CHECK_INT_EQ(vf_convergence_next_run(&b->convergence, 4, 0.0), 3);
  vf_film_destroy(a);
  vf_film_destroy(b);
  vf_film_destroy(c);
}

static void test_film_file_keeps_log_scene_and_cpu_time(void) {
  const char *path = fixture_path("log.exr"), *bad = fixture_path("bad.exr");
  vf_film *f = synthetic_film(8, 5, 0, 4), *back = NULL;
  if (!f) return;
  vf_convergence_entry e[2] = {entry(0, 0.75, 3, NAN, 0.5), entry(0, 1.0, 4, 0.3125, 0.375)};
  for (int i = 0; i < 2; i++) vf_convergence_append(&f->convergence, &e[i]);
  snprintf(f->scene_name, sizeof f->scene_name, "/some/where/box.json");
  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
  if (back) {
    CHECK_INT_EQ(back->convergence.count, 2);
    for (size_t i = 0; i < 2 && i < back->convergence.count; i++) CHECK(entries_equal(&back->convergence.entries[i], &e[i]));
    CHECK(strcmp(back->scene_name, f->scene_name) == 0);
    CHECK_NEAR(back->cpu_seconds, f->cpu_seconds, 0);
    CHECK_NEAR(vf_film_estimate_rmse(back), vf_film_estimate_rmse(f), 1e-12 * vf_film_estimate_rmse(f));
  }
  vf_film_destroy(back);
  back = NULL;

  /* damage the log in place (same length): refused, naming the attribute */
  size_t size = 0;
  unsigned char *bytes = fixture_slurp(path, &size);
  unsigned char *at = bytes ? memmem(bytes, size, "0 0.75 1.5 3 nan nan 0.5\n", 25) : NULL;
  CHECK(at != NULL);
  if (at) {
    memcpy(at, "0 0.75 1.5 3 nan nan -.5\n", 25);
    fixture_spill(bad, bytes, size);
    int err = vf_film_read(bad, &back);
    CHECK_INT_EQ(err, VF_EFILM);
    CHECK_STR_CONTAINS(vf_error_detail(err), "vcmfarm:convergence");
    CHECK_STR_CONTAINS(vf_error_detail(err), bad);
    CHECK(back == NULL);
  }
  free(bytes);
  unlink(path);
  unlink(bad);
  vf_film_destroy(f);
}

/* ---- the estimate against the truth on cornell ---- */

#define EST_SIZE 64
#define REF_ITERATIONS 4096
#define REF_SEED 777

static vf_film *render_film(const vf_scene *scene, vf_algorithm algorithm, vf_sampler_kind sampler, uint64_t seed,
                            uint64_t begin, uint64_t end, vf_film *into) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.sampler = sampler;
  s.seed = seed;
  s.width = s.height = EST_SIZE;
  vf_renderer *r = NULL;
  vf_film *film = into;
  CHECK_INT_EQ(vf_renderer_create(scene, &s, 0, &r), VF_OK);
  if (film == NULL && vf_film_create(s.width, s.height, &film) == VF_OK) vf_renderer_stamp(r, film);
  if (r && film) CHECK_INT_EQ(vf_render_range(r, film, begin, end, NULL, NULL), VF_OK);
  vf_renderer_destroy(r);
  return film;
}

/* The reference has independent numbers, whose estimate has long been checked (the film's
 * square sums then are squares). It is expensive (~30 s on 2 cores), so it is cached in the build directory
 * under a name made of its settings; a cached film is used only if its scene hash, settings
 * and iteration set are exactly those asked for. Never committed. */
static vf_film *reference_film(const vf_scene *scene) {
  char dir[512], path[1024];
  snprintf(dir, sizeof dir, "%s/test-cache", VF_BINARY_DIR);
  mkdir(dir, 0777);
  snprintf(path, sizeof path, "%s/reference-cornell-bpt-seed%d-%dx%d-%d.exr", dir, REF_SEED, EST_SIZE, EST_SIZE,
           REF_ITERATIONS);
  vf_film *ref = NULL;
  if (vf_film_read(path, &ref) == VF_OK) {
    vf_film *probe = render_film(scene, VF_ALGO_BPT, VF_SAMPLER_INDEPENDENT, REF_SEED, 0, 0, NULL); /* stamped, empty */
    int ok = probe && memcmp(probe->scene_hash, ref->scene_hash, 32) == 0 &&
             strcmp(probe->settings_text, ref->settings_text) == 0 && ref->iterations.count == 1 &&
             ref->iterations.ranges[0].begin == 0 && ref->iterations.ranges[0].end == REF_ITERATIONS;
    vf_film_destroy(probe);
    if (ok) {
      printf("  reference: cached %s\n", path);
      return ref;
    }
    vf_film_destroy(ref);
  }
  printf("  reference: rendering %d bpt iterations (seed %d) into %s\n", REF_ITERATIONS, REF_SEED, path);
  fflush(stdout);
  ref = render_film(scene, VF_ALGO_BPT, VF_SAMPLER_INDEPENDENT, REF_SEED, 0, REF_ITERATIONS, NULL);
  if (ref) vf_film_write(ref, path);
  return ref;
}

/* true MSE of film = E|I - truth|^2 ~ mean|I - R|^2 - (R's own MSE), the two being
 * independent (other algorithm, other seed); R's MSE is its own estimate, 1/16 of the film's
 * at 256 iterations, so even a rough value of it changes little. */
static double true_rmse(const vf_film *film, const vf_film *ref, const float *ref_mean) {
  size_t n = 3 * (size_t)film->width * (size_t)film->height;
  float *mean = malloc(n * sizeof *mean);
  vf_film_mean(film, mean);
  double se = 0.0;
  for (size_t i = 0; i < n; i++) se += ((double)mean[i] - ref_mean[i]) * ((double)mean[i] - ref_mean[i]);
  free(mean);
  double ref_est = vf_film_estimate_rmse(ref);
  return sqrt(fmax(se / (double)n - ref_est * ref_est, 0.0));
}

static void test_estimate_matches_true_rmse_on_cornell(void) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (!scene) return;
  vf_film *ref = reference_film(scene);
  if (!ref) return;
  float *ref_mean = malloc(3 * (size_t)ref->width * (size_t)ref->height * sizeof *ref_mean);
  vf_film_mean(ref, ref_mean);
  static const vf_algorithm algorithms[] = {VF_ALGO_VCM, VF_ALGO_PT};
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++)
    for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
      vf_sampler_kind sampler = (vf_sampler_kind)k;
      vf_film *film = render_film(scene, algorithms[a], sampler, 1, 0, 16, NULL);
      if (!film) break;
      for (int stage = 0; stage < 2; stage++) {
        if (stage == 1) render_film(scene, algorithms[a], sampler, 1, 16, 256, film);
        double est = vf_film_estimate_rmse(film), truth = true_rmse(film, ref, ref_mean);
        double factor = est / truth;
        printf("  %-3s %-11s %3d iterations: estimated RMSE %.5f, true RMSE %.5f (reference's own %.5f): factor "
               "%.3f\n",
               vf_algorithm_name(algorithms[a]), vf_sampler_name(sampler), stage ? 256 : 16, est, truth,
               vf_film_estimate_rmse(ref), factor);
        CHECK(factor >= 1.0 / 1.5 && factor <= 1.5);
      }
      vf_film_destroy(film);
    }
  free(ref_mean);
  vf_film_destroy(ref);
  vf_scene_destroy(scene);
}

int main(void) {
  if (fixture_scratch_open("test_convergence") != 0) return 1;
  RUN(test_log_text_round_trips);
  RUN(test_malformed_log_text_is_refused);
  RUN(test_estimate_is_the_standard_error_of_the_mean);
  RUN(test_sobol_estimate_is_the_spread_of_the_replicates);
  RUN(test_merge_appends_the_source_log_as_new_runs);
  RUN(test_film_file_keeps_log_scene_and_cpu_time);
  RUN(test_estimate_matches_true_rmse_on_cornell);
  fixture_scratch_close();
  return check_finish();
}
