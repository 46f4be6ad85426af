/* Numerical stability under stress (issue 5, section 3): the renderer must give the same
 * image at any scene scale, with extreme materials and lights, and never let a NaN or Inf
 * reach an accumulator. Every check is against physics or another run of the renderer at a
 * benign setting, never against stored pixels. */
#include "check.h"
#include "render_util.h"
#include "worker/scene/builtin.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"

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
  /* Renders start at `first`, and their error bars come from the spread of the iterations:
   * independent numbers (the sobol sampler's error bars need independent seeds,
   * render_block_estimates). */
  s.sampler = VF_SAMPLER_INDEPENDENT;
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

static const vf_algorithm algorithms[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_PT,  VF_ALGO_LT,
                                          VF_ALGO_PPM, VF_ALGO_BPM, VF_ALGO_UPG};

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

/* A small open scene: a floor, a patch lying on it `gap` above (nearly coincident when the
 * gap is tiny), two spheres touching each other and the floor's patch, an area light,
 * degenerate and sliver triangles in the floor mesh, and a camera placed by the caller. */
static vf_scene *extreme_scene(double gap, const char *camera, const char *floor_material) {
  char text[4096];
  double y = gap;
  snprintf(text, sizeof text,
           "{\"camera\": %s,"
           " \"materials\": {\"floor\": %s, \"patch\": {\"diffuse\": [0.7, 0.2, 0.2]},"
           "   \"ball\": {\"diffuse\": [0.2, 0.5, 0.7], \"glossy\": [0.3, 0.3, 0.3], \"exponent\": 100000},"
           "   \"lamp\": {}},"
           " \"shapes\": ["
           "  {\"type\": \"mesh\", \"material\": \"floor\", \"positions\": [-2,0,-2, 2,0,-2, 2,0,2, -2,0,2,"
           "    0,0,0, 1,0,0, 2,0,0, -2,0,1, 2,0,1.00001, 2,0,1.00002],"
           "   \"indices\": [0,2,1, 0,3,2, 4,5,6, 7,9,8]},"
           "  {\"type\": \"mesh\", \"material\": \"patch\", \"positions\": [-1,%.17g,-1, 0,%.17g,-1, 0,%.17g,0, -1,%.17g,0],"
           "   \"indices\": [0,2,1, 0,3,2]},"
           "  {\"type\": \"sphere\", \"material\": \"ball\", \"center\": [0.5, 0.4, -0.5], \"radius\": 0.4},"
           "  {\"type\": \"sphere\", \"material\": \"ball\", \"center\": [1.3, 0.4, -0.5], \"radius\": 0.4},"
           "  {\"type\": \"mesh\", \"material\": \"lamp\", \"emission\": [6, 6, 6],"
           "   \"positions\": [-0.5,2.5,-0.5, 0.5,2.5,-0.5, 0.5,2.5,0.5, -0.5,2.5,0.5, 0,2.5,0, 0.1,2.5,0, 0.2,2.5,0],"
           "   \"indices\": [0,1,2, 0,2,3, 4,5,6]}],"
           " \"lights\": [{\"type\": \"background\", \"radiance\": [0.2, 0.2, 0.25]}]}",
           camera, floor_material, y, y, y, y);
  vf_scene *scene = NULL;
  CHECK_INT_EQ(vf_scene_parse(text, strlen(text), "extreme", ".", NULL, 0, &scene), VF_OK);
  return scene;
}

static const char *front_camera = "{\"position\": [0, 1.5, 4], \"target\": [0, 0.2, 0], \"fov\": 50}";

/* A patch 1e-6 of the scene's size above the floor renders as a patch 1e-3 above it does:
 * no floor showing through (z-fighting), no light leaking through the gap, no acne. The
 * same scene holds touching spheres, Phong exponent 1e5, a zero-area triangle in the
 * emitter, zero-area and sliver triangles in the floor. */
static void test_nearly_coincident_surfaces_and_degenerate_geometry(void) {
  const char *diffuse_floor = "{\"diffuse\": [0.6, 0.6, 0.6]}";
  vf_scene *near = extreme_scene(4e-6, front_camera, diffuse_floor);
  vf_scene *far = extreme_scene(4e-3, front_camera, diffuse_floor);
  if (near == NULL || far == NULL) return;
  const vf_algorithm some[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_PT};
  for (int a = 0; a < 3; a++) {
    estimate e_near, e_far;
    CHECK_INT_EQ(render_estimate(near, some[a], 21, 0, 0, &e_near), VF_OK);
    CHECK_INT_EQ(render_estimate(far, some[a], 22, 0, 0, &e_far), VF_OK);
    char what[96];
    snprintf(what, sizeof what, "gap 1e-6 vs 1e-3, %s", vf_algorithm_name(some[a]));
    check_same_image(what, &e_near, &e_far, 1.0);
  }
  vf_scene_destroy(near);
  vf_scene_destroy(far);
}

/* A camera 1e-4 above the floor looking along it: nearly every hit is at a grazing angle.
 * The algorithms must agree with each other, and nothing may be NaN or Inf. */
static void test_grazing_camera(void) {
  vf_scene *s = extreme_scene(1e-3, "{\"position\": [-1.9, 0.0001, 1.9], \"target\": [1.9, 0.0001, -1.9], \"fov\": 30}",
                              "{\"diffuse\": [0.3, 0.3, 0.3], \"glossy\": [0.5, 0.5, 0.5], \"exponent\": 20}");
  if (s == NULL) return;
  estimate pt, vcm;
  CHECK_INT_EQ(render_estimate(s, VF_ALGO_PT, 31, 0, 0, &pt), VF_OK);
  CHECK_INT_EQ(render_estimate(s, VF_ALGO_VCM, 32, 0, 0, &vcm), VF_OK);
  check_same_image("grazing camera, vcm vs pt", &vcm, &pt, 1.0);
  vf_scene_destroy(s);
}

/* Glass of index 1.0001 (almost invisible) and 3.0 (strong reflection, total internal
 * reflection): every algorithm agrees with path tracing on cornell with either glass. */
static void test_extreme_indices_of_refraction(void) {
  const float iors[] = {1.0001f, 3.0f};
  for (int i = 0; i < 2; i++) {
    vf_scene *s;
    CHECK_INT_EQ(vf_scene_load("cornell", &s), VF_OK);
    if (check_failed_in_case) return;
    for (int m = 0; m < s->num_materials; m++)
      if (!vf_is_zero(s->materials[m].dielectric)) s->materials[m].ior = iors[i];
    estimate pt, vcm, bpt;
    CHECK_INT_EQ(render_estimate(s, VF_ALGO_PT, 41, 0, 0, &pt), VF_OK);
    CHECK_INT_EQ(render_estimate(s, VF_ALGO_VCM, 42, 0, 0, &vcm), VF_OK);
    CHECK_INT_EQ(render_estimate(s, VF_ALGO_BPT, 43, 0, 0, &bpt), VF_OK);
    char what[96];
    snprintf(what, sizeof what, "cornell glass ior %g, vcm vs pt", iors[i]);
    check_same_image(what, &vcm, &pt, 1.0);
    snprintf(what, sizeof what, "cornell glass ior %g, bpt vs pt", iors[i]);
    check_same_image(what, &bpt, &pt, 1.0);
    vf_scene_destroy(s);
  }
}

int main(void) {
  RUN(test_scene_scale_leaves_the_image_unchanged);
  RUN(test_light_power_extremes_scale_the_image_linearly);
  RUN(test_iteration_1e9_merges_vanish_gracefully);
  RUN(test_path_length_100_in_the_furnace);
  RUN(test_nearly_coincident_surfaces_and_degenerate_geometry);
  RUN(test_grazing_camera);
  RUN(test_extreme_indices_of_refraction);
  return check_finish();
}
