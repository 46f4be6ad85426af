/* Numerical stability under stress (issue 5, section 3): the renderer must give the same
 * image at any scene scale, with extreme materials and lights, and never let a NaN or Inf
 * reach an accumulator. Every check is against physics or another run of the renderer at a
 * benign setting, never against stored pixels. */
#include "check.h"
#include "render_util.h"

#include <string.h>

enum { RES = 64, BLOCKS = 4, NB = BLOCKS * BLOCKS, ITERATIONS = 48 };

typedef struct {
  double mean[NB], se[NB];
  uint64_t nonfinite;
} estimate;

static int render_estimate(const vf_scene *scene, vf_algorithm algorithm, uint64_t seed, uint64_t first, int max_path,
                           estimate *e) {
  vf_settings s = scene->settings;
  s.algorithm = algorithm;
  s.width = s.height = RES;
  s.seed = seed;
  if (max_path > 0) s.max_path_length = max_path;
  static double means[ITERATIONS * NB];
  vf_vcm_stats stats = {0};
  int err = render_block_means(scene, &s, 2, first, ITERATIONS, BLOCKS, means, &stats);
  for (int b = 0; b < NB; b++) mean_and_standard_error(means, ITERATIONS, NB, b, &e->mean[b], &e->se[b]);
  e->nonfinite = stats.nonfinite;
  return err;
}

/* Independent estimates agree: every block within 5 combined standard errors and mean z^2
 * near 1, after scaling b by `factor` (an exact multiplier of the image). */
static void check_same_image(const char *what, const estimate *a, const estimate *b, double factor) {
  double max_z = 0.0, sum_z2 = 0.0;
  for (int k = 0; k < NB; k++) {
    double d = a->mean[k] - factor * b->mean[k];
    double se = sqrt(a->se[k] * a->se[k] + factor * factor * b->se[k] * b->se[k]);
    double z = se > 0.0 ? d / se : (d == 0.0 ? 0.0 : INFINITY);
    max_z = fmax(max_z, fabs(z));
    sum_z2 += z * z;
  }
  printf("  %-44s max |z| %5.2f, mean z^2 %5.2f, non-finite %llu/%llu\n", what, max_z, sum_z2 / NB,
         (unsigned long long)a->nonfinite, (unsigned long long)b->nonfinite);
  CHECK(max_z < 5.0);
  CHECK(sum_z2 / NB < 2.5);
  CHECK_INT_EQ(a->nonfinite, 0);
  CHECK_INT_EQ(b->nonfinite, 0);
}

static const vf_algorithm algorithms[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_PPM, VF_ALGO_BPM};

/* The whole scene scaled by S (point lights adjusted) is the same image. */
static void test_scene_scale_leaves_the_image_unchanged(void) {
  const double scales[] = {1e-4, 1e-2, 1e2, 1e4};
  const char *scenes[] = {"cornell", "cornell-point"};
  for (int sc = 0; sc < 2; sc++)
    for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
      vf_scene *base;
      CHECK_INT_EQ(vf_scene_load(scenes[sc], &base), VF_OK);
      if (check_failed_in_case) return;
      estimate reference;
      CHECK_INT_EQ(render_estimate(base, algorithms[a], 1, 0, 0, &reference), VF_OK);
      for (int i = 0; i < 4; i++) {
        vf_scene *scaled;
        CHECK_INT_EQ(vf_scene_load(scenes[sc], &scaled), VF_OK);
        CHECK_INT_EQ(vf_scene_scale(scaled, scales[i]), VF_OK);
        estimate e;
        CHECK_INT_EQ(render_estimate(scaled, algorithms[a], 2 + (uint64_t)i, 0, 0, &e), VF_OK);
        char what[96];
        snprintf(what, sizeof what, "%s %s scale %g", scenes[sc], vf_algorithm_name(algorithms[a]), scales[i]);
        check_same_image(what, &e, &reference, 1.0);
        vf_scene_destroy(scaled);
      }
      vf_scene_destroy(base);
    }
}

/* Radiance is linear: lights 1e-6 and 1e6 times as bright give the image times 1e-6 and
 * 1e6, with nothing underflowing or overflowing on the way. */
static void test_light_power_extremes_scale_the_image_linearly(void) {
  const float factors[] = {1e-6f, 1e6f};
  vf_scene *base;
  CHECK_INT_EQ(vf_scene_load("cornell", &base), VF_OK);
  if (check_failed_in_case) return;
  for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
    estimate reference;
    CHECK_INT_EQ(render_estimate(base, algorithms[a], 1, 0, 0, &reference), VF_OK);
    for (int i = 0; i < 2; i++) {
      vf_scene *s;
      CHECK_INT_EQ(vf_scene_load("cornell", &s), VF_OK);
      for (int k = 0; k < s->num_shapes; k++) s->shapes[k].emission = vf_scale(s->shapes[k].emission, factors[i]);
      estimate e;
      CHECK_INT_EQ(render_estimate(s, algorithms[a], 7, 0, 0, &e), VF_OK);
      char what[96];
      snprintf(what, sizeof what, "cornell %s emission x %g", vf_algorithm_name(algorithms[a]), factors[i]);
      check_same_image(what, &e, &reference, factors[i]);
      vf_scene_destroy(s);
    }
  }
  vf_scene_destroy(base);
}

/* A huge iteration index shrinks the merge radius to almost nothing: the merging weights
 * must vanish gracefully (no overflow into Inf or NaN), leaving the connection techniques
 * to carry the image, which then agrees with BPT. */
static void test_iteration_1e9_merges_vanish_gracefully(void) {
  vf_scene *s;
  CHECK_INT_EQ(vf_scene_load("cornell", &s), VF_OK);
  if (check_failed_in_case) return;
  estimate vcm, bpt;
  CHECK_INT_EQ(render_estimate(s, VF_ALGO_VCM, 3, 1000000000ULL, 0, &vcm), VF_OK);
  CHECK_INT_EQ(render_estimate(s, VF_ALGO_BPT, 4, 1000000000ULL, 0, &bpt), VF_OK);
  check_same_image("cornell vcm vs bpt at iteration 1e9", &vcm, &bpt, 1.0);
  vf_scene_destroy(s);
}

/* Long paths: maximum path length 100 in the furnace, whose exact value is 1 - 0.5^100. */
static void test_path_length_100_in_the_furnace(void) {
  vf_scene *s;
  CHECK_INT_EQ(vf_scene_load("furnace", &s), VF_OK);
  if (check_failed_in_case) return;
  for (size_t a = 0; a < sizeof algorithms / sizeof *algorithms; a++) {
    estimate e;
    CHECK_INT_EQ(render_estimate(s, algorithms[a], 5, 0, 100, &e), VF_OK);
    double mean = 0.0, var = 0.0;
    for (int b = 0; b < NB; b++) {
      mean += e.mean[b] / NB;
      var += e.se[b] * e.se[b] / ((double)NB * NB);
    }
    printf("  furnace %-4s L=100: mean %.5f +- %.5f\n", vf_algorithm_name(algorithms[a]), mean, sqrt(var));
    CHECK_NEAR(mean, 1.0, 4.0 * sqrt(var) + 1e-6);
    CHECK_INT_EQ(e.nonfinite, 0);
  }
  vf_scene_destroy(s);
}

int main(void) {
  RUN(test_scene_scale_leaves_the_image_unchanged);
  RUN(test_light_power_extremes_scale_the_image_linearly);
  RUN(test_iteration_1e9_merges_vanish_gracefully);
  RUN(test_path_length_100_in_the_furnace);
  return check_finish();
}
