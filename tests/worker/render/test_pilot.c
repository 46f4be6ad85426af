/* Camera sub-paths allocated per pixel from a pilot (--pilot, common/allocation.h).
 *
 * Physics: with any allocation (here a fixed pattern of 1 to 16 camera sub-paths a pixel,
 * and the one a pilot computes) pt, bpt and vcm keep the furnace's analytic value and
 * agree block by block with bpt of one camera sub-path a pixel, on the box with a mirror
 * and a glass ball (light tracing's share weighed against k camera sub-paths) and on the
 * glossy box; merging's bias at a large fixed radius falls, not grows, when the pixels
 * trace more camera sub-paths (their radius shrinks with their count); the film's own
 * error estimate stays within 1.5 times the error two independent films show. The render loop's promises: the allocation a pilot computes is
 * the same on 1 and 2 threads and from the pilot's film merged from parts; a film with an
 * allocation continues (through its file) and merges bit for bit as one rendered in one
 * go; films of other allocations refuse to merge; a damaged allocation in a file is
 * refused; auto with a pilot chooses by the candidates' pilots, and the allocation it
 * hands on is the chosen one's own, or the pixels' choice between bpt and vcm, each pixel of
 * which renders as its own algorithm does. The MIS identity with k camera sub-paths a pixel is
 * test_mis's test_weights_match_eq12_with_camera_sub_paths_allocated_per_pixel. */
#include "check.h"
#include "common/allocation.h"
#include "common/error.h"
#include "common/film.h"
#include "render_util.h"
#include "worker/render/render.h"
#include "worker/scene/load.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static vf_sampler_kind sampler_under_test = VF_SAMPLER_SOBOL;

/* A fixed allocation of every count: pixel (x, y) traces 2^((x / 3 + y) mod 5). */
static uint8_t *pattern(int width, int height) {
  uint8_t *samples = malloc((size_t)width * height);
  if (samples == NULL) return NULL;
  for (int y = 0; y < height; y++)
    for (int x = 0; x < width; x++) samples[(size_t)y * width + x] = (uint8_t)(1u << ((x / 3 + y) % 5));
  return samples;
}

/* The furnace: every path of up to L segments sees 1 - 0.5^L, however many camera
 * sub-paths a pixel traces. */
static void test_furnace_gives_the_analytic_value(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  uint8_t *samples = pattern(scene->settings.width, scene->settings.height);
  render_allocation = samples;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  for (int a = 0; a < 3; a++) {
    vf_settings s = scene->settings;
    s.algorithm = algorithms[a];
    s.pilot = 8;
    s.sampler = sampler_under_test;
    vf_vcm_stats stats = {0};
    double mean = NAN, se = NAN;
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, 32, 1, &mean, &se, &stats), VF_OK);
    double exact = 1.0 - pow(0.5, s.max_path_length);
    printf("  furnace %-3s %-11s mean %.5f +- %.5f (exact %.5f)\n", vf_algorithm_name(s.algorithm),
           vf_sampler_name(s.sampler), mean, se, exact);
    CHECK_NEAR(mean, exact, 3.0 * se);
    CHECK(se < 0.005);
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  render_allocation = NULL;
  free(samples);
  vf_scene_destroy(scene);
}

#ifdef __SANITIZE_ADDRESS__
enum { RES = 32, ITERATIONS = 32 }; /* memory errors, not statistics: agreement printed only */
#define AGREE(x) ((void)(x))
#else
enum { RES = 64, ITERATIONS = 128 };
#define AGREE(x) CHECK(x)
#endif
enum { BLOCKS = 8, NB = BLOCKS * BLOCKS };

/* Block means and standard errors of `iterations` iterations of `algorithm` with the
 * allocation `samples` (NULL: none), at RES x RES. */
static void block_estimates_n(const vf_scene *scene, vf_algorithm algorithm, const uint8_t *samples, int iterations,
                              double mean[NB], double se[NB]) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.pilot = samples ? 8 : 0;
  s.width = s.height = RES;
  s.seed = 7000 + 10 * (uint64_t)algorithm + (samples != NULL);
  s.sampler = sampler_under_test;
  vf_vcm_stats stats = {0};
  render_allocation = samples;
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, iterations, BLOCKS, mean, se, &stats), VF_OK);
  render_allocation = NULL;
  CHECK_INT_EQ(stats.nonfinite, 0);
}

static void block_estimates(const vf_scene *scene, vf_algorithm algorithm, const uint8_t *samples, double mean[NB],
                            double se[NB]) {
  block_estimates_n(scene, algorithm, samples, ITERATIONS, mean, se);
}

/* The allocation a pilot of `pilot` iterations computes for `settings` on `threads`
 * threads (NULL on failure), from the film vf_render_pilot gives. */
static uint8_t *pilot_allocation(const vf_scene *scene, const vf_settings *settings, int threads) {
  vf_renderer *r = NULL;
  vf_film *film = NULL;
  uint8_t *samples = NULL;
  CHECK_INT_EQ(vf_renderer_create(scene, settings, threads, &r), VF_OK);
  CHECK_INT_EQ(vf_film_create(settings->width, settings->height, &film), VF_OK);
  if (r && film) {
    CHECK_INT_EQ(vf_renderer_stamp(r, film), VF_OK);
    CHECK_INT_EQ(vf_render_pilot(r, film, NULL, NULL), VF_OK);
    CHECK(film->samples != NULL);
    if (film->samples) {
      samples = film->samples;
      film->samples = NULL;
    }
  }
  vf_film_destroy(film);
  vf_renderer_destroy(r);
  return samples;
}

/* pt, bpt and vcm with the pattern's 1 to 16 camera sub-paths a pixel against bpt of one:
 * on cornell (a mirror and a glass ball: light tracing carries the caustics, and its
 * weight against k camera sub-paths decides their share) and, with the allocation its
 * pilot computes, on the glossy box. */
static void test_allocations_agree_with_one_camera_sub_path(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (check_failed_in_case) return;
  uint8_t *samples = pattern(RES, RES);
  double ref[NB], ref_se[NB], x[NB], x_se[NB];
  block_estimates(scene, VF_ALGO_BPT, NULL, ref, ref_se);
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  for (int a = 0; a < 3; a++) {
    block_estimates(scene, algorithms[a], samples, x, x_se);
    AGREE(blocks_agree("cornell k", "bpt", vf_algorithm_name(algorithms[a]), ref, ref_se, x, x_se, NB));
  }
  free(samples);
  vf_scene_destroy(scene);

  CHECK_INT_EQ(vf_scene_load("cornell-glossy", &scene), VF_OK);
  if (check_failed_in_case) return;
  block_estimates(scene, VF_ALGO_BPT, NULL, ref, ref_se);
  vf_settings s = scene->settings;
  s.algorithm = VF_ALGO_VCM;
  s.pilot = 16;
  s.width = s.height = RES;
  s.sampler = sampler_under_test;
  samples = pilot_allocation(scene, &s, 2);
  if (samples) {
    vf_allocation_report report;
    vf_allocation_describe(samples, (size_t)RES * RES, &report);
    printf("  glossy pilot: %.2f camera sub-paths a pixel; of 1, 2, 4, 8, 16: %llu %llu %llu %llu %llu\n", report.mean,
           (unsigned long long)report.pixels[0], (unsigned long long)report.pixels[1],
           (unsigned long long)report.pixels[2], (unsigned long long)report.pixels[3],
           (unsigned long long)report.pixels[4]);
    CHECK(report.pixels[0] < (uint64_t)RES * RES); /* the pilot allocated something */
    block_estimates(scene, VF_ALGO_VCM, samples, x, x_se);
    AGREE(blocks_agree("glossy pilot", "bpt", "vcm", ref, ref_se, x, x_se, NB));
    block_estimates(scene, VF_ALGO_BPT, samples, x, x_se);
    AGREE(blocks_agree("glossy pilot", "bpt", "bpt", ref, ref_se, x, x_se, NB));
  }
  free(samples);
  vf_scene_destroy(scene);
}

/* The mean over the blocks of a's squared bias against b, (a - b)^2 less both
 * variances, and its standard error into se (of d^2 for a Gaussian difference d). */
static double squared_bias(const double *a, const double *se_a, const double *b, const double *se_b, double *se) {
  double sum = 0.0, var = 0.0;
  for (int k = 0; k < NB; k++) {
    double d = a[k] - b[k], s2 = se_a[k] * se_a[k] + se_b[k] * se_b[k];
    sum += d * d - s2;
    var += 4.0 * d * d * s2 + 2.0 * s2 * s2;
  }
  *se = sqrt(var) / NB;
  return sum / NB;
}

/* Merging's bias does not grow with the allocation (worker/render/pixel_radius.h): a pixel
 * of k camera sub-paths merges with radius r / sqrt(k), so that merging's count falls by k
 * as light tracing's does. At a large fixed radius (0.05 of the scene's, alpha 1) on the
 * box with a rough glass ball, whose caustic on the floor light tracing and merging share,
 * vcm's squared bias per block against bpt (the blocks' d^2 - se_a^2 - se_b^2, averaged)
 * must fall when every pixel traces 4 camera sub-paths: each merge's kernel is half as
 * wide and merging's share no larger. With the radius kept, merging took the caustic over
 * from light tracing and the squared bias grew (measured: 1.25 times k = 1's; with r / 2,
 * 0.35 times). The case at k = 1 must show a bias, or the test would have no power. */
static void test_merging_bias_does_not_grow_with_the_allocation(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell-rough", &scene), VF_OK);
  uint8_t *four = malloc((size_t)RES * RES);
  if (scene == NULL || four == NULL) goto done;
  scene->settings.radius_factor = 0.05;
  scene->settings.alpha = 1.0;
  memset(four, 4, (size_t)RES * RES);
  double ref[NB], ref_se[NB], one[NB], one_se[NB], k4[NB], k4_se[NB], se1, se4, mean = 0.0;
  block_estimates_n(scene, VF_ALGO_BPT, NULL, 4 * ITERATIONS, ref, ref_se);
  block_estimates_n(scene, VF_ALGO_VCM, NULL, 4 * ITERATIONS, one, one_se);
  block_estimates_n(scene, VF_ALGO_VCM, four, 4 * ITERATIONS, k4, k4_se);
  double b1 = squared_bias(one, one_se, ref, ref_se, &se1), b4 = squared_bias(k4, k4_se, ref, ref_se, &se4);
  for (int k = 0; k < NB; k++) mean += ref[k] / NB;
  printf("  vcm's squared bias per block against bpt over the mean squared: one camera sub-path %.3g +- %.2g, four "
         "%.3g +- %.2g\n",
         b1 / (mean * mean), se1 / (mean * mean), b4 / (mean * mean), se4 / (mean * mean));
  AGREE(b1 > 5.0 * se1);             /* a bias to lose */
  AGREE(b4 < 0.5 * b1 + 3.0 * se4); /* lost in part, beyond the noise */
done:
  free(four);
  vf_scene_destroy(scene);
}

/* A job of `algorithm` on cornell at 40x30 with a pilot of 8. */
static vf_settings job(const vf_scene *scene, vf_algorithm algorithm) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.pilot = 8;
  s.width = 40;
  s.height = 30;
  s.seed = 21;
  s.sampler = sampler_under_test;
  return s;
}

/* Iterations [begin, end) of the job into film (which gets its allocation from the pilot
 * first if it has none), on `threads` threads. */
static void render_into(const vf_scene *scene, const vf_settings *s, vf_film *film, int threads, uint64_t begin,
                        uint64_t end) {
  vf_renderer *r = NULL;
  CHECK_INT_EQ(vf_renderer_create(scene, s, threads, &r), VF_OK);
  if (r == NULL) return;
  if (film->settings_text[0] == '\0') CHECK_INT_EQ(vf_renderer_stamp(r, film), VF_OK);
  CHECK_INT_EQ(vf_render_pilot(r, film, NULL, NULL), VF_OK);
  CHECK_INT_EQ(vf_render_range(r, film, begin, end, NULL, NULL), VF_OK);
  vf_renderer_destroy(r);
}

static vf_film *new_film(const vf_settings *s) {
  vf_film *film = NULL;
  CHECK_INT_EQ(vf_film_create(s->width, s->height, &film), VF_OK);
  return film;
}

/* The allocation is a pure function of the pilot's film: 1 and 2 threads, and the pilot's
 * parts [0,3) and [3,8) merged, give the same counts. */
static void test_the_allocation_is_the_same_however_the_pilot_ran(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (check_failed_in_case) return;
  vf_settings s = job(scene, VF_ALGO_VCM);
  size_t n = (size_t)s.width * s.height;
  uint8_t *one = pilot_allocation(scene, &s, 1), *two = pilot_allocation(scene, &s, 2);
  vf_renderer *r = NULL;
  vf_film *a = new_film(&s), *b = new_film(&s);
  uint8_t *split = malloc(n);
  CHECK_INT_EQ(vf_renderer_create(scene, &s, 2, &r), VF_OK);
  if (one && two && r && a && b && split) {
    CHECK_INT_EQ(vf_renderer_stamp(r, a), VF_OK);
    CHECK_INT_EQ(vf_renderer_stamp(r, b), VF_OK);
    CHECK_INT_EQ(vf_render_pilot_range(r, a, 3, 8, NULL, NULL), VF_OK);
    CHECK_INT_EQ(vf_render_pilot_range(r, b, 0, 3, NULL, NULL), VF_OK);
    /* The pilot is the pilot's: its iterations are not the job's. */
    CHECK_INT_EQ(vf_render_pilot_range(r, b, 8, 9, NULL, NULL), VF_EINVAL);
    CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
    CHECK_INT_EQ(vf_allocation_compute(a, split, NULL), VF_OK);
    vf_allocation_report report;
    vf_allocation_describe(one, n, &report);
    int threads = memcmp(one, two, n) == 0, parts = memcmp(one, split, n) == 0;
    printf("  %-11s %.2f camera sub-paths a pixel; 1 vs 2 threads %s, [0,3) + [3,8) vs [0,8) %s\n",
           vf_sampler_name(sampler_under_test), report.mean, threads ? "equal" : "DIFFER", parts ? "equal" : "DIFFER");
    CHECK(threads);
    CHECK(parts);
    CHECK(report.mean > 1.0);
    /* Only the pilot's whole film decides: a part of it is refused. */
    CHECK_INT_EQ(vf_allocation_compute(b, split, NULL), VF_EINVAL);
  }
  vf_renderer_destroy(r);
  vf_film_destroy(a);
  vf_film_destroy(b);
  free(one);
  free(two);
  free(split);
  vf_scene_destroy(scene);
}

/* A film with an allocation: [0,6) in one go against [0,2) written, read back and continued
 * to 6, and against [0,3) and [3,6) rendered apart (each running the pilot) and merged, bit
 * for bit, for pt, bpt and vcm. A film of another allocation does not merge with it, nor
 * one without a pilot. */
static void test_continues_and_merges_exactly(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (check_failed_in_case) return;
  const vf_algorithm algorithms[] = {VF_ALGO_PT, VF_ALGO_BPT, VF_ALGO_VCM};
  char path[] = "/tmp/vf_test_pilot_XXXXXX";
  int fd = mkstemp(path);
  CHECK(fd >= 0);
  if (fd >= 0) close(fd);
  for (int i = 0; i < 3 && !check_failed_in_case; i++) {
    vf_settings s = job(scene, algorithms[i]);
    vf_film *whole = new_film(&s), *first = new_film(&s), *a = new_film(&s), *b = new_film(&s), *read = NULL;
    if (!whole || !first || !a || !b) break;
    render_into(scene, &s, whole, 2, 0, 6);
    render_into(scene, &s, first, 1, 0, 2);
    CHECK_INT_EQ(vf_film_write(first, path), VF_OK);
    CHECK_INT_EQ(vf_film_read(path, &read), VF_OK);
    if (read) render_into(scene, &s, read, 2, 2, 6);
    render_into(scene, &s, a, 2, 0, 3);
    render_into(scene, &s, b, 1, 3, 6);
    CHECK_INT_EQ(vf_film_merge(b, a), VF_OK);
    int continued = read && films_bitwise_equal(read, whole), merged = films_bitwise_equal(b, whole);
    printf("  %-3s %-11s [0,2) written, read, continued to 6: %s; [0,3) + [3,6): %s\n", vf_algorithm_name(s.algorithm),
           vf_sampler_name(s.sampler), continued ? "equal" : "DIFFER", merged ? "equal" : "DIFFER");
    CHECK(continued);
    CHECK(merged);
    CHECK(strstr(whole->settings_text, " pilot=8") != NULL);
    /* Another allocation (one pixel's count changed): refused, dst unchanged. */
    vf_film *other = NULL;
    CHECK_INT_EQ(vf_film_clone(first, &other), VF_OK);
    if (other) {
      vf_iterset_destroy(&other->iterations);
      vf_iterset_init(&other->iterations);
      CHECK_INT_EQ(vf_iterset_add(&other->iterations, 6, 7), VF_OK);
      other->samples[0] = other->samples[0] == 1 ? 2 : 1;
      CHECK_INT_EQ(vf_film_merge(whole, other), VF_EMISMATCH);
      CHECK(films_bitwise_equal(b, whole));
      vf_film_destroy(other);
    }
    /* Without a pilot: other settings. */
    vf_settings plain = s;
    plain.pilot = 0;
    vf_film *none = new_film(&plain);
    if (none) {
      render_into(scene, &plain, none, 2, 6, 7);
      CHECK(none->samples == NULL);
      CHECK_INT_EQ(vf_film_merge(whole, none), VF_EMISMATCH);
      vf_film_destroy(none);
    }
    vf_film_destroy(whole);
    vf_film_destroy(first);
    vf_film_destroy(a);
    vf_film_destroy(b);
    vf_film_destroy(read);
  }
  unlink(path);
  vf_scene_destroy(scene);
}

/* Sums of camera and light images per pixel over the iterations render_iterations gives. */
typedef struct {
  size_t pixels;
  double *sum;
} pixel_sums;

static void add_pixel_sums(void *ctx, int i, const float *cam, const float *light) {
  (void)i;
  pixel_sums *p = ctx;
  for (size_t k = 0; k < 3 * p->pixels; k++) p->sum[k] += (double)cam[k] + (double)light[k];
}

/* Iterations [0, 3) of s with allocation `samples` into 3 x pixels sums (calloc'ed). */
static double *sums_with(const vf_scene *scene, const vf_settings *s, const uint8_t *samples) {
  pixel_sums p = {(size_t)s->width * s->height, calloc(3 * (size_t)s->width * s->height, sizeof(double))};
  if (p.sum == NULL) return NULL;
  render_allocation = samples;
  vf_vcm_stats stats = {0};
  CHECK_INT_EQ(render_iterations(scene, s, 2, 0, 3, add_pixel_sums, &p, &stats), VF_OK);
  CHECK_INT_EQ(stats.nonfinite, 0);
  render_allocation = NULL;
  return p.sum;
}

/* Merging per pixel (allocation.h, VF_ALLOCATION_NO_MERGING): a vcm render whose
 * allocation turns merging off in some pixels renders each of those pixels exactly as bpt
 * does and every other pixel exactly as vcm does, from the same sub-paths (every technique
 * of a path weighs it by its pixel's merge parameters, pixel_radius.h), so that each
 * pixel's estimator is one of two the other tests prove; and the two differ, or the test
 * would show nothing. On the box with a mirror and a glass ball (caustics, which merging
 * carries), counts of 1 to 16 and merging off on a checkerboard of 5 x 5 pixels. Its film
 * continues through its file bit for bit. Only vcm takes such an allocation. */
static void test_merging_per_pixel_is_bpt_or_vcm_pixel_by_pixel(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (check_failed_in_case) return;
  vf_settings vcm = job(scene, VF_ALGO_VCM), bpt = job(scene, VF_ALGO_BPT);
  size_t n = (size_t)vcm.width * vcm.height;
  uint8_t *counts = pattern(vcm.width, vcm.height), *mixed = malloc(n);
  if (counts == NULL || mixed == NULL) goto done;
  size_t off = 0;
  for (int y = 0; y < vcm.height; y++)
    for (int x = 0; x < vcm.width; x++) {
      size_t p = (size_t)y * vcm.width + x;
      int flagged = (x / 5 + y / 5) % 2;
      mixed[p] = (uint8_t)(counts[p] | (flagged ? VF_ALLOCATION_NO_MERGING : 0u));
      off += (size_t)flagged;
    }
  double *m = sums_with(scene, &vcm, mixed), *v = sums_with(scene, &vcm, counts), *b = sums_with(scene, &bpt, counts);
  if (m && v && b) {
    size_t unequal = 0, differ = 0;
    double worst = 0.0;
    for (size_t p = 0; p < n; p++) {
      const double *own = vf_allocation_merges(mixed[p]) ? v : b;
      for (size_t c = 3 * p; c < 3 * p + 3; c++) {
        double d = fabs(m[c] - own[c]) / fmax(fabs(own[c]), 1e-3);
        worst = fmax(worst, d);
        unequal += d > 1e-5;
      }
      differ += fabs(v[3 * p] - b[3 * p]) > 1e-3 * fmax(fabs(b[3 * p]), 1e-3);
    }
    printf("  %-11s %zu of %zu pixels without merging: each pixel as its own algorithm's, largest relative difference "
           "%.2g (%zu channels above 1e-5); vcm and bpt differ in %zu pixels\n",
           vf_sampler_name(vcm.sampler), off, n, worst, unequal, differ);
    CHECK_INT_EQ(unequal, 0);
    CHECK(differ > n / 4);
  }
  free(m);
  free(v);
  free(b);
  /* Its film keeps the flags: [0,2) written, read back and continued to 4 is [0,4) in one
   * go, bit for bit. */
  char path[] = "/tmp/vf_test_pilot_mixed_XXXXXX";
  int fd = mkstemp(path);
  CHECK(fd >= 0);
  if (fd >= 0) close(fd);
  vf_film *whole = new_film(&vcm), *first = new_film(&vcm), *read = NULL;
  if (whole && first) {
    CHECK_INT_EQ(vf_film_set_samples(whole, mixed), VF_OK);
    CHECK_INT_EQ(vf_film_set_samples(first, mixed), VF_OK);
    render_into(scene, &vcm, whole, 2, 0, 4);
    render_into(scene, &vcm, first, 1, 0, 2);
    CHECK_INT_EQ(vf_film_write(first, path), VF_OK);
    CHECK_INT_EQ(vf_film_read(path, &read), VF_OK);
    if (read) {
      CHECK(memcmp(read->samples, mixed, n) == 0);
      render_into(scene, &vcm, read, 2, 2, 4);
      CHECK(films_bitwise_equal(read, whole));
    }
  }
  unlink(path);
  vf_film_destroy(whole);
  vf_film_destroy(first);
  vf_film_destroy(read);
  /* bpt (or any but vcm) refuses an allocation that turns merging off. */
  vf_accel *accel = NULL;
  vf_pool *pool = NULL;
  vf_vcm *r = NULL;
  bpt.pilot = 8;
  CHECK_INT_EQ(vf_accel_create(scene, &accel), VF_OK);
  CHECK_INT_EQ(vf_pool_create(1, &pool), VF_OK);
  CHECK_INT_EQ(vf_vcm_create(scene, accel, &bpt, pool, &r), VF_OK);
  if (r) {
    CHECK_INT_EQ(vf_vcm_set_allocation(r, mixed), VF_EINVAL);
    CHECK(strstr(vf_error_detail(VF_EINVAL), "only a vcm render") != NULL);
    CHECK_INT_EQ(vf_vcm_set_allocation(r, counts), VF_OK);
  }
  vf_vcm_destroy(r);
  vf_pool_destroy(pool);
  vf_accel_destroy(accel);
done:
  free(counts);
  free(mixed);
  vf_scene_destroy(scene);
}

/* vf_allocation_choose: a tile's pixels merge unless bpt's variance times its cost, times
 * the margin, is at most vcm's over the tile; the counts follow each pixel's own variance
 * over its cost. (A row of 64 pixels: four tiles.) */
static void test_merging_is_chosen_where_it_pays(void) {
  enum { N = 64 };
  double vb[N], vv[N];
  uint8_t samples[N];
  for (int p = 0; p < N; p++) {
    vb[p] = 1.0;
    vv[p] = p < 16 ? 0.1 : p < 32 ? 1.2 : 2.0; /* 10x better, within the margin, worse */
  }
  vf_allocation_report report;
  CHECK_INT_EQ(vf_allocation_choose(vb, vv, 1e-6, 1e-6, 1.25, N, 1, samples, &report), VF_OK);
  int right = 1;
  for (int p = 0; p < N; p++) right &= vf_allocation_merges(samples[p]) == (p < 32);
  CHECK(right);
  CHECK_INT_EQ(report.no_merging, 32);
  /* sqrt(v / c): a merging pixel (v 0.1) gets fewer camera sub-paths than a bpt one (v 1). */
  CHECK(vf_allocation_count(samples[0]) < vf_allocation_count(samples[40]));
  CHECK_INT_EQ(vf_allocation_validate(samples, N, "chosen"), VF_OK);
  /* At 20 times the cost merging pays nowhere, at a twentieth everywhere. */
  CHECK_INT_EQ(vf_allocation_choose(vb, vv, 1e-6, 2e-5, 1.25, N, 1, samples, &report), VF_OK);
  CHECK_INT_EQ(report.no_merging, N);
  CHECK_INT_EQ(vf_allocation_choose(vb, vv, 1e-6, 5e-8, 1.25, N, 1, samples, &report), VF_OK);
  CHECK_INT_EQ(report.no_merging, 0);
  CHECK_INT_EQ(vf_allocation_choose(vb, vv, 0.0, 1e-6, 1.25, N, 1, samples, &report), VF_EINVAL);
  /* 32 x 32 pixels, four tiles: the left two merge (vcm 10 times better), the right two do
   * not (2 times worse); one pixel of the left ones, 3 times worse, does not decide alone. */
  enum { S = 32 };
  double b2[S * S], v2[S * S];
  uint8_t tiles[S * S];
  for (int p = 0; p < S * S; p++) {
    b2[p] = 1.0;
    v2[p] = p % S < 16 ? 0.1 : 2.0;
  }
  v2[3 * S + 3] = 3.0;
  CHECK_INT_EQ(vf_allocation_choose(b2, v2, 1e-6, 1e-6, 1.25, S, S, tiles, &report), VF_OK);
  int by_tile = 1;
  for (int p = 0; p < S * S; p++) by_tile &= vf_allocation_merges(tiles[p]) == (p % S < 16);
  CHECK(by_tile);
  /* The flag survives a film's text; the unused bits are refused. */
  for (int p = 0; p < N; p++) samples[p] = (uint8_t)((1u << (p % 5)) | (p % 2 ? VF_ALLOCATION_NO_MERGING : 0u));
  char *text = NULL;
  uint8_t back[N];
  CHECK_INT_EQ(vf_allocation_encode(samples, N, &text), VF_OK);
  if (text) CHECK_INT_EQ(vf_allocation_decode(text, N, back, "f.exr"), VF_OK);
  CHECK(memcmp(samples, back, N) == 0);
  free(text);
  samples[9] = 0x40 | 2;
  CHECK_INT_EQ(vf_allocation_validate(samples, N, "f.exr"), VF_EFILM);
  CHECK(strstr(vf_error_detail(VF_EFILM), "pixel 9") != NULL);
  samples[9] = VF_ALLOCATION_NO_MERGING; /* no count */
  CHECK_INT_EQ(vf_allocation_validate(samples, N, "f.exr"), VF_EFILM);
}

/* vcmfarm:allocation as a file keeps it (allocation.h): bad text is refused by name. */
static void test_a_damaged_allocation_is_refused(void) {
  enum { N = 1000 };
  uint8_t samples[N], back[N];
  for (int i = 0; i < N; i++) samples[i] = (uint8_t)(1u << (i * 7 % 5));
  char *text = NULL;
  CHECK_INT_EQ(vf_allocation_encode(samples, N, &text), VF_OK);
  if (text == NULL) return;
  CHECK_INT_EQ(vf_allocation_decode(text, N, back, "f.exr"), VF_OK);
  CHECK(memcmp(samples, back, N) == 0);
  CHECK_INT_EQ(vf_allocation_decode(text, N - 1, back, "f.exr"), VF_EFILM); /* another size */
  CHECK(strstr(vf_error_detail(VF_EFILM), "f.exr") != NULL);
  CHECK_INT_EQ(vf_allocation_decode(text + 2, N, back, "f.exr"), VF_EFILM); /* no version */
  char *bad = strdup(text);
  if (bad) {
    bad[5] = '*'; /* not base64 */
    CHECK_INT_EQ(vf_allocation_decode(bad, N, back, "f.exr"), VF_EFILM);
    free(bad);
  }
  free(text);
  samples[17] = 3; /* not a power of two */
  CHECK_INT_EQ(vf_allocation_encode(samples, N, &text), VF_OK);
  if (text) CHECK_INT_EQ(vf_allocation_decode(text, N, back, "f.exr"), VF_EFILM);
  free(text);
}

/* The film's error estimate with the allocation a pilot computes: two films of other
 * seeds differ by sqrt(2) times the true RMSE (bpt is unbiased); each one's estimate must
 * be within 1.5 times that. */
static void test_the_estimate_covers_the_error(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell-glossy", &scene), VF_OK);
  if (check_failed_in_case) return;
  vf_settings s = scene->settings;
  s.algorithm = VF_ALGO_BPT;
  s.pilot = 16;
  s.width = s.height = RES;
  s.sampler = sampler_under_test;
  vf_film *f[2] = {NULL, NULL};
  for (int i = 0; i < 2; i++) {
    s.seed = 31 + (uint64_t)i;
    f[i] = new_film(&s);
    if (f[i]) render_into(scene, &s, f[i], 2, 0, ITERATIONS);
  }
  if (f[0] && f[1]) {
    size_t n = (size_t)RES * RES;
    float *m0 = malloc(3 * n * sizeof *m0), *m1 = malloc(3 * n * sizeof *m1);
    if (m0 && m1) {
      vf_film_mean(f[0], m0);
      vf_film_mean(f[1], m1);
      double d2 = 0.0;
      for (size_t i = 0; i < 3 * n; i++) d2 += ((double)m0[i] - m1[i]) * ((double)m0[i] - m1[i]);
      double rmse = sqrt(d2 / (3.0 * (double)n) / 2.0);
      for (int i = 0; i < 2; i++) {
        double est = vf_film_estimate_rmse(f[i]);
        printf("  %-11s estimate %.5f, true RMSE (from the pair) %.5f: ratio %.2f\n", vf_sampler_name(s.sampler), est,
               rmse, est / rmse);
        AGREE(est / rmse < 1.5 && rmse / est < 1.5);
      }
    }
    free(m0);
    free(m1);
  }
  vf_film_destroy(f[0]);
  vf_film_destroy(f[1]);
  vf_scene_destroy(scene);
}

/* auto with a pilot: the pilots of pt, bpt and vcm measured, the most efficient chosen (pt
 * over a margin);
 * on the lamp in a glass ball, whose light pt reaches only through emission hits along
 * specular chains, not pt. The chosen one's allocation is the one its own pilot gives
 * (here on one thread, there on two), so the job's film is that algorithm's, bit for bit. */
static void test_auto_chooses_by_its_pilots(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell-bulb", &scene), VF_OK);
  if (check_failed_in_case) return;
  vf_settings s = job(scene, VF_ALGO_AUTO);
  uint8_t *samples = malloc((size_t)s.width * s.height);
  vf_auto_choice choice;
  CHECK_INT_EQ(vf_render_choose_algorithm(scene, &s, 2, NULL, samples, &choice), VF_OK);
  CHECK(choice.count == 3 || choice.count == 4);
  int best = 0;
  for (int i = 0; i < choice.count; i++) {
    double merging = choice.candidates[i].merging;
    printf("  %s (merging in %.1f%% of pixels): efficiency %.4g, %.2f camera sub-paths a pixel, variance %.4g, "
           "%.2f + %.2f ms an iteration\n",
           vf_algorithm_name(choice.candidates[i].algorithm), 100.0 * merging, choice.candidates[i].efficiency,
           choice.candidates[i].camera_subpaths, choice.candidates[i].variance,
           1e3 * choice.candidates[i].light_seconds, 1e3 * choice.candidates[i].camera_seconds);
    CHECK(choice.candidates[i].efficiency > 0.0 && choice.candidates[i].efficiency < 1e300);
    CHECK(choice.candidates[i].camera_subpaths >= 1.0 && choice.candidates[i].camera_subpaths <= VF_ALLOCATION_MAX);
    /* pt over the margin, bpt and vcm (merging everywhere or per tile) as they are */
    double margin = choice.candidates[i].algorithm == VF_ALGO_PT ? VF_AUTO_MARGIN : 1.0;
    double best_margin = choice.candidates[best].algorithm == VF_ALGO_PT ? VF_AUTO_MARGIN : 1.0;
    if (choice.candidates[i].efficiency / margin > choice.candidates[best].efficiency / best_margin) best = i;
  }
  CHECK_INT_EQ(choice.candidates[0].algorithm, VF_ALGO_PT);
  CHECK_INT_EQ(choice.candidates[1].algorithm, VF_ALGO_BPT);
  CHECK_INT_EQ(choice.candidates[2].algorithm, VF_ALGO_VCM);
  if (choice.count == 4) {
    CHECK_INT_EQ(choice.candidates[3].algorithm, VF_ALGO_VCM);
    CHECK(choice.candidates[3].merging > 0.0 && choice.candidates[3].merging < 1.0);
  }
  CHECK_INT_EQ(choice.chosen, best);
  CHECK_INT_EQ(choice.algorithm, choice.candidates[best].algorithm);
  CHECK_INT_EQ(s.algorithm, choice.algorithm);
  CHECK(s.algorithm != VF_ALGO_PT);
  CHECK(choice.render_seconds > 0.0);
  size_t n = (size_t)s.width * s.height, off = 0;
  for (size_t p = 0; samples && p < n; p++) off += !vf_allocation_merges(samples[p]);
  if (best < 3) {
    /* One algorithm: its own pilot's allocation. */
    uint8_t *own = pilot_allocation(scene, &s, 1);
    CHECK(own != NULL && samples != NULL && memcmp(own, samples, n) == 0);
    free(own);
  } else {
    /* Merging per pixel: the flags say where, as the candidate's share. */
    CHECK(samples != NULL && off > 0 && off < n);
    CHECK_NEAR(1.0 - (double)off / (double)n, choice.candidates[3].merging, 1e-12);
  }
  free(samples);
  /* Only auto with a pilot is chosen so. */
  vf_settings plain = job(scene, VF_ALGO_AUTO);
  plain.pilot = 0;
  CHECK_INT_EQ(vf_render_choose_algorithm(scene, &plain, 1, NULL, NULL, &choice), VF_EINVAL);
  vf_settings fixed = job(scene, VF_ALGO_BPT);
  CHECK_INT_EQ(vf_render_choose_algorithm(scene, &fixed, 1, NULL, NULL, &choice), VF_EINVAL);
  vf_scene_destroy(scene);
}

/* No pilot is the default and writes no key; a pilot of 1, one of lt, ppm, bpm, upg or of
 * single-stage vcm is refused with the reason. */
static void test_settings(void) {
  vf_settings s;
  vf_settings_default(&s);
  CHECK_INT_EQ(s.pilot, 0);
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK(strstr(text, "pilot") == NULL);
  s.pilot = 16;
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  vf_settings back;
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK_INT_EQ(back.pilot, 16);
  s.pilot = 1;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
  s.pilot = 8;
  const vf_algorithm refused[] = {VF_ALGO_LT, VF_ALGO_PPM, VF_ALGO_BPM, VF_ALGO_UPG, VF_ALGO_AUTO_UNBIASED};
  for (int i = 0; i < 5; i++) {
    s.algorithm = refused[i];
    CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
    CHECK(strstr(vf_error_detail(VF_EINVAL), "pilot") != NULL);
  }
  s.algorithm = VF_ALGO_VCM;
  s.vcm_stages = 1;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
}

int main(void) {
  RUN(test_settings);
  RUN(test_a_damaged_allocation_is_refused);
  RUN(test_merging_is_chosen_where_it_pays);
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    sampler_under_test = (vf_sampler_kind)k;
    printf("sampler %s\n", vf_sampler_name(sampler_under_test));
    RUN(test_furnace_gives_the_analytic_value);
    RUN(test_the_allocation_is_the_same_however_the_pilot_ran);
    RUN(test_continues_and_merges_exactly);
    RUN(test_merging_per_pixel_is_bpt_or_vcm_pixel_by_pixel);
  }
  /* The statistics once, with the default sampler: the other's numbers have been through
   * the furnace and the promises above. */
  sampler_under_test = VF_SAMPLER_SOBOL;
  RUN(test_allocations_agree_with_one_camera_sub_path);
  RUN(test_merging_bias_does_not_grow_with_the_allocation);
  RUN(test_the_estimate_covers_the_error);
  RUN(test_auto_chooses_by_its_pilots);
  return check_finish();
}
