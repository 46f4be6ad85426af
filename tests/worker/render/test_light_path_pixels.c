/* Fewer light sub-paths than pixels (--light-path-pixels N, common/settings.h): blocks of
 * N pixels share the light sub-path their top-left pixel traces, and n_light counts the
 * blocks. Physics: the furnace's analytic value and agreement with pt block by block for
 * vcm (two-stage and single-stage), bpt and lt, so that light tracing's 1 / n_light,
 * merging's eta = pi r^2 n_light and the connections to a shared sub-path are all right;
 * the render loop's promises (1 and 2 threads, split ranges) bit for bit, on an image whose
 * sides no block divides; and N = 1 is the default. The MIS identity with
 * n_light below the pixels is test_mis's test_weights_match_eq12_with_fewer_light_paths_than_pixels. */
#include "check.h"
#include "common/error.h"
#include "common/film.h"
#include "render_util.h"
#include "worker/render/render.h"
#include "worker/scene/load.h"

#include <stdlib.h>
#include <string.h>

static vf_sampler_kind sampler_under_test = VF_SAMPLER_SOBOL;

/* The furnace: every path of up to L segments sees 1 - 0.5^L, whatever shares a light
 * sub-path. */
static void test_furnace_gives_the_analytic_value(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  const struct {
    vf_algorithm a;
    int stages, pixels;
  } cases[] = {{VF_ALGO_VCM, 2, 8}, {VF_ALGO_VCM, 1, 8}, {VF_ALGO_VCM, 2, 64}, {VF_ALGO_BPT, 2, 8}, {VF_ALGO_LT, 2, 8}};
  for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
    vf_settings s = scene->settings;
    s.algorithm = cases[i].a;
    s.vcm_stages = cases[i].stages;
    s.light_path_pixels = cases[i].pixels;
    s.sampler = sampler_under_test;
    vf_vcm_stats stats = {0};
    double mean = NAN, se = NAN;
    CHECK_INT_EQ(render_block_estimates(scene, &s, 2, 64, 1, &mean, &se, &stats), VF_OK);
    double exact = 1.0 - pow(0.5, s.max_path_length);
    printf("  furnace %-3s stages %d, %2d pixels a light sub-path, %-11s mean %.5f +- %.5f (exact %.5f)\n",
           vf_algorithm_name(s.algorithm), s.vcm_stages, s.light_path_pixels, vf_sampler_name(s.sampler), mean, se,
           exact);
    CHECK_NEAR(mean, exact, 3.0 * se);
    /* lt has light tracing alone, through an eighth of the light sub-paths */
    CHECK(se < (s.algorithm == VF_ALGO_LT ? 0.01 : 0.005));
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  vf_scene_destroy(scene);
}

#ifdef __SANITIZE_ADDRESS__
enum { RES = 64 };
#else
enum { RES = 128 };
#endif
enum { BLOCKS = 8, NB = BLOCKS * BLOCKS, ITERATIONS = 128 };

static void block_estimates(const vf_scene *scene, vf_algorithm algorithm, int stages, int pixels, double mean[NB],
                            double se[NB], vf_vcm_stats *stats) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.vcm_stages = stages;
  s.light_path_pixels = pixels;
  s.width = s.height = RES;
  s.seed = 6000 + 10 * (uint64_t)algorithm + (uint64_t)stages + 100 * (uint64_t)pixels;
  s.sampler = sampler_under_test;
  *stats = (vf_vcm_stats){0};
  CHECK_INT_EQ(render_block_estimates(scene, &s, 2, ITERATIONS, BLOCKS, mean, se, stats), VF_OK);
  CHECK_INT_EQ(stats->nonfinite, 0);
}

/* With area lights pt estimates the image alone; vcm (both stages) and bpt with 8 pixels a
 * light sub-path, and lt with 4 on the diffuse box (its only technique: every pixel's value
 * comes through the blocks' light sub-paths), must agree with it block by block. cornell has a mirror and a
 * glass ball, whose caustics merging and light tracing carry. The stored light vertices
 * fall with the light sub-paths: one 4x2 block of 8 pixels traces one. */
static void test_fewer_light_paths_agree_with_pt(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (check_failed_in_case) return;
  double pt[NB], pt_se[NB], x[NB], x_se[NB];
  vf_vcm_stats stats, all;
  block_estimates(scene, VF_ALGO_PT, 2, 1, pt, pt_se, &stats);
  block_estimates(scene, VF_ALGO_VCM, 2, 8, x, x_se, &stats);
  CHECK(blocks_agree("cornell /8", "pt", "vcm", pt, pt_se, x, x_se, NB));
  block_estimates(scene, VF_ALGO_VCM, 1, 8, x, x_se, &stats);
  CHECK(blocks_agree("cornell /8", "pt", "vcm1", pt, pt_se, x, x_se, NB));
  block_estimates(scene, VF_ALGO_BPT, 2, 8, x, x_se, &stats);
  CHECK(blocks_agree("cornell /8", "pt", "bpt", pt, pt_se, x, x_se, NB));
  block_estimates(scene, VF_ALGO_VCM, 2, 1, x, x_se, &all);
  block_estimates(scene, VF_ALGO_VCM, 2, 8, x, x_se, &stats);
  double ratio = (double)all.light_vertices / (double)stats.light_vertices;
  printf("  light vertices stored, one light sub-path a pixel over one per 8 pixels: %.2f\n", ratio);
  CHECK(ratio > 6.0 && ratio < 10.0);
  vf_scene_destroy(scene);
  /* lt samples no path that meets the camera through the mirror or the glass: on the
   * diffuse box it samples every path. */
  if (sampler_under_test != VF_SAMPLER_SOBOL) return; /* lt's blocks are heavy-tailed: once */
  CHECK_INT_EQ(vf_scene_load("cornell-diffuse", &scene), VF_OK);
  if (check_failed_in_case) return;
  block_estimates(scene, VF_ALGO_PT, 2, 1, pt, pt_se, &stats);
  block_estimates(scene, VF_ALGO_LT, 2, 4, x, x_se, &stats);
  CHECK(blocks_agree("diffuse /4", "pt", "lt", pt, pt_se, x, x_se, NB));
  vf_scene_destroy(scene);
}

/* Iterations [begin, end) of vcm into a film, on `threads` threads, at 90x70: no block of
 * 8x8 or 4x2 divides the sides, the last tiles are cut. */
static vf_film *render(int stages, int pixels, int threads, uint64_t begin, uint64_t end) {
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_load("cornell", &scene), VF_OK);
  if (scene == NULL) return NULL;
  vf_settings s = scene->settings;
  s.algorithm = VF_ALGO_VCM;
  s.vcm_stages = stages;
  s.light_path_pixels = pixels;
  s.sampler = sampler_under_test;
  s.seed = 11;
  s.width = 90;
  s.height = 70;
  vf_film *film = render_film(scene, &s, threads, begin, end);
  vf_scene_destroy(scene);
  return film;
}

/* Every iteration stays a pure function of (seed, global index, path index): 1 and 2
 * threads, and [0,1) + [1,3) + [3,5) against [0,5), bit for bit, both stages. */
static void test_reproducible_and_splits_exactly(void) {
  const int pixels[] = {8, 64};
  for (int stages = 1; stages <= 2; stages++)
    for (int p = 0; p < 2; p++) {
      vf_film *one = render(stages, pixels[p], 1, 0, 3), *two = render(stages, pixels[p], 2, 0, 3);
      vf_film *whole = render(stages, pixels[p], 2, 0, 5);
      vf_film *a = render(stages, pixels[p], 2, 0, 1), *b = render(stages, pixels[p], 1, 1, 3),
              *d = render(stages, pixels[p], 2, 3, 5);
      if (!one || !two || !whole || !a || !b || !d) return;
      CHECK(strstr(whole->settings_text, " light_path_pixels=") != NULL);
      CHECK_INT_EQ(vf_film_merge(d, b), VF_OK);
      CHECK_INT_EQ(vf_film_merge(d, a), VF_OK);
      int threads = films_bitwise_equal(one, two), split = films_bitwise_equal(d, whole);
      printf("  stages %d, %2d pixels, %-11s 1 vs 2 threads %s; [0,1) + [1,3) + [3,5) vs [0,5): %s\n", stages,
             pixels[p], vf_sampler_name(sampler_under_test), threads ? "equal" : "DIFFER", split ? "equal" : "DIFFER");
      CHECK(threads);
      CHECK(split);
      vf_film_destroy(one);
      vf_film_destroy(two);
      vf_film_destroy(whole);
      vf_film_destroy(a);
      vf_film_destroy(b);
      vf_film_destroy(d);
    }
}

/* N = 1 is the default and writes no key into the settings text (so that every film of
 * before reads as it); a film of another N does not merge with it. */
static void test_one_pixel_a_light_path_is_the_default(void) {
  vf_film *dflt = render(2, 1, 2, 0, 2), *eight = render(2, 8, 2, 2, 4);
  if (!dflt || !eight) return;
  CHECK(strstr(dflt->settings_text, "light_path_pixels") == NULL);
  vf_settings s;
  vf_settings_default(&s);
  CHECK_INT_EQ(s.light_path_pixels, 1);
  CHECK_INT_EQ(vf_film_merge(dflt, eight), VF_EMISMATCH);
  vf_film_destroy(dflt);
  vf_film_destroy(eight);
}

int main(void) {
  RUN(test_one_pixel_a_light_path_is_the_default);
  for (int k = 0; k < VF_SAMPLER_COUNT_; k++) {
    sampler_under_test = (vf_sampler_kind)k;
    printf("sampler %s\n", vf_sampler_name(sampler_under_test));
    RUN(test_furnace_gives_the_analytic_value);
    RUN(test_reproducible_and_splits_exactly);
#ifdef __SANITIZE_ADDRESS__
    if (sampler_under_test != VF_SAMPLER_SOBOL) continue; /* memory errors, not statistics */
#endif
    RUN(test_fewer_light_paths_agree_with_pt);
  }
  return check_finish();
}
