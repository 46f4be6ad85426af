/* Physics of the whole renderer: the furnace and the agreement of independent algorithms. */
#include "check.h"
#include "render_util.h"

static const vf_algorithm all_algorithms[] = {VF_ALGO_VCM, VF_ALGO_BPT, VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_PPM, VF_ALGO_BPM};

/* A closed enclosure of albedo a whose walls all emit Le: every path of up to L segments
 * sees Le (1 + a + ... + a^(L-1)) = Le (1 - a^L) / (1 - a), which is 1 - 0.5^L here. */
static void test_furnace_every_algorithm_gives_the_analytic_value(void) {
  vf_scene *scene;
  CHECK_INT_EQ(vf_scene_load("furnace", &scene), VF_OK);
  if (check_failed_in_case) return;
  enum { N = 64 };
  for (size_t a = 0; a < sizeof all_algorithms / sizeof *all_algorithms; a++) {
    vf_settings s = scene->settings;
    s.algorithm = all_algorithms[a];
    double means[N];
    vf_vcm_stats stats = {0};
    CHECK_INT_EQ(render_block_means(scene, &s, 2, 0, N, 1, means, &stats), VF_OK);
    double mean, se;
    mean_and_standard_error(means, N, 1, 0, &mean, &se);
    double exact = 1.0 - pow(0.5, s.max_path_length);
    printf("  furnace %-4s mean %.5f +- %.5f (exact %.5f), %llu non-finite\n", vf_algorithm_name(s.algorithm), mean, se,
           exact, (unsigned long long)stats.nonfinite);
    CHECK_NEAR(mean, exact, 3.0 * se);
    CHECK(se < 0.005); /* the check above must have teeth */
    CHECK_INT_EQ(stats.nonfinite, 0);
  }
  vf_scene_destroy(scene);
}

int main(void) {
  RUN(test_furnace_every_algorithm_gives_the_analytic_value);
  return check_finish();
}
