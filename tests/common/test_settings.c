/* Render settings' canonical text (common/settings.h): what a film and a farm job carry,
 * and what decides whether two films may merge. */
#include "check.h"

#include "common/error.h"
#include "common/settings.h"

#include <string.h>

static void test_text_round_trips(void) {
  vf_settings s, back;
  vf_settings_default(&s);
  s.alpha = 0.6;
  s.radius_factor = 0.01;
  s.mis_beta = 2.5;
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, " mis_beta=2.5");
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK(back.mis_beta == 2.5 && back.alpha == 0.6 && back.radius_factor == 0.01 && back.sampler == s.sampler);
}

/* Every text written before the power heuristic existed was rendered with the balance
 * heuristic: it has no mis_beta and reads as 1, and a film of beta 1 writes none, so the
 * two still merge; a film of another beta never does (its text differs). */
static void test_balance_heuristic_is_the_text_without_beta(void) {
  vf_settings s;
  const char *old = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3 sampler=sobol";
  CHECK_INT_EQ(vf_settings_parse(&s, old), VF_OK);
  CHECK(s.mis_beta == 1.0);
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK(strcmp(text, old) == 0);
}

static void test_beta_out_of_range_or_twice_is_refused(void) {
  vf_settings s;
  const char *base = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3";
  const char *bad[] = {" mis_beta=0.5", " mis_beta=4.5", " mis_beta=nan", " mis_beta=2x", " mis_beta=2 mis_beta=2"};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    char text[512];
    snprintf(text, sizeof text, "%s%s", base, bad[i]);
    int err = vf_settings_parse(&s, text);
    if (err != VF_EINVAL) CHECK_FAIL_("'%s' parsed (%d)", bad[i], err);
  }
  vf_settings_default(&s);
  s.mis_beta = VF_MAX_MIS_BETA;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_OK);
  s.mis_beta = 0.999;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "MIS beta");
}

/* upg's side: written only when it is the camera's (every text before it existed gathered
 * from no side and reads as the light's), read back, refused twice or for another
 * algorithm; auto-unbiased and upg read back as themselves. */
static void test_gather_side_and_new_algorithms(void) {
  vf_settings s, back;
  vf_settings_default(&s);
  s.algorithm = VF_ALGO_UPG;
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, "algorithm=upg ");
  CHECK(strstr(text, "gather") == NULL);
  s.gather = VF_GATHER_CAMERA;
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, " gather=camera");
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK(back.gather == VF_GATHER_CAMERA && back.algorithm == VF_ALGO_UPG);
  const char *base = "algorithm=upg max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3";
  const char *bad[] = {" gather=eye", " gather=camera gather=camera", " gather="};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    snprintf(text, sizeof text, "%s%s", base, bad[i]);
    int err = vf_settings_parse(&back, text);
    if (err != VF_EINVAL) CHECK_FAIL_("'%s' parsed (%d)", bad[i], err);
  }
  s.algorithm = VF_ALGO_VCM;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "option of upg");
  vf_algorithm a;
  CHECK_INT_EQ(vf_algorithm_parse("auto-unbiased", &a), VF_OK);
  CHECK(a == VF_ALGO_AUTO_UNBIASED && vf_algorithm_is_auto(a));
  CHECK(vf_algorithm_estimate_scope(VF_ALGO_UPG) == VF_ESTIMATE_ERROR);
  CHECK(vf_algorithm_estimate_scope(VF_ALGO_AUTO_UNBIASED) == VF_ESTIMATE_ERROR);
  CHECK(vf_algorithm_estimate_scope(VF_ALGO_VCM) == VF_ESTIMATE_VARIANCE);
  CHECK(vf_algorithm_estimate_scope(VF_ALGO_AUTO) == VF_ESTIMATE_DEPENDS);
}

/* The stages of vcm: written only when single-stage (every text before it existed was
 * two-stage), read back, refused twice, out of range, or for an algorithm other than vcm
 * and auto. */
/* Pixels sharing a light sub-path: written only when not 1 (every text before it existed
 * had one light sub-path a pixel), read back, refused twice, when not a power of two up to
 * the largest, and for pt and upg. */
static void test_light_path_pixels(void) {
  vf_settings s, back;
  vf_settings_default(&s);
  CHECK_INT_EQ(s.light_path_pixels, 1);
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK(strstr(text, "light_path_pixels") == NULL);
  s.light_path_pixels = 8;
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, " light_path_pixels=8");
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK_INT_EQ(back.light_path_pixels, 8);
  const char *base = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3";
  const char *bad[] = {" light_path_pixels=3", " light_path_pixels=0", " light_path_pixels=2048",
                       " light_path_pixels=-4", " light_path_pixels=4 light_path_pixels=4", " light_path_pixels=",
                       " light_path_pixels=8x", " light_path_pixels=4294967304"};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    snprintf(text, sizeof text, "%s%s", base, bad[i]);
    int err = vf_settings_parse(&back, text);
    if (err != VF_EINVAL) CHECK_FAIL_("'%s' parsed (%d)", bad[i], err);
  }
  s.light_path_pixels = 1024;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_OK);
  const vf_algorithm fine[] = {VF_ALGO_BPT, VF_ALGO_LT, VF_ALGO_PPM, VF_ALGO_BPM, VF_ALGO_AUTO};
  for (size_t i = 0; i < sizeof fine / sizeof *fine; i++) {
    s.algorithm = fine[i];
    CHECK_INT_EQ(vf_settings_validate(&s), VF_OK);
  }
  s.algorithm = VF_ALGO_PT;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
  s.algorithm = VF_ALGO_UPG;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "not of upg");
}

static void test_vcm_stages(void) {
  vf_settings s, back;
  vf_settings_default(&s);
  CHECK_INT_EQ(s.vcm_stages, 2);
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK(strstr(text, "vcm_stages") == NULL);
  s.vcm_stages = 1;
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, " vcm_stages=1");
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK_INT_EQ(back.vcm_stages, 1);
  const char *base = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3";
  const char *bad[] = {" vcm_stages=3", " vcm_stages=0", " vcm_stages=1 vcm_stages=1", " vcm_stages=", " vcm_stages=1x"};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    snprintf(text, sizeof text, "%s%s", base, bad[i]);
    int err = vf_settings_parse(&back, text);
    if (err != VF_EINVAL) CHECK_FAIL_("'%s' parsed (%d)", bad[i], err);
  }
  s.algorithm = VF_ALGO_AUTO;
  CHECK_INT_EQ(vf_settings_validate(&s), VF_OK);
  const vf_algorithm other[] = {VF_ALGO_BPT, VF_ALGO_PT, VF_ALGO_LT, VF_ALGO_UPG, VF_ALGO_PPM, VF_ALGO_BPM,
                                VF_ALGO_AUTO_UNBIASED};
  for (size_t i = 0; i < sizeof other / sizeof *other; i++) {
    s.algorithm = other[i];
    CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "single-stage");
  }
}

/* The merge radius: written only when per pixel (every text before it existed had one
 * radius), read back, refused twice, unknown, or for an algorithm that does not merge. */
static void test_radius_per_pixel(void) {
  vf_settings s, back;
  vf_settings_default(&s);
  char text[512];
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK(strstr(text, "radius=") == NULL);
  s.radius = VF_RADIUS_PER_PIXEL;
  CHECK_INT_EQ(vf_settings_format(&s, text, sizeof text), VF_OK);
  CHECK_STR_CONTAINS(text, " radius=per-pixel");
  CHECK_INT_EQ(vf_settings_parse(&back, text), VF_OK);
  CHECK(back.radius == VF_RADIUS_PER_PIXEL);
  const char *base = "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=4x3";
  const char *bad[] = {" radius=local", " radius=per-pixel radius=per-pixel", " radius="};
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    snprintf(text, sizeof text, "%s%s", base, bad[i]);
    int err = vf_settings_parse(&back, text);
    if (err != VF_EINVAL) CHECK_FAIL_("'%s' parsed (%d)", bad[i], err);
  }
  const vf_algorithm merging[] = {VF_ALGO_VCM, VF_ALGO_UPG, VF_ALGO_PPM, VF_ALGO_BPM, VF_ALGO_AUTO, VF_ALGO_AUTO_UNBIASED};
  for (size_t i = 0; i < sizeof merging / sizeof *merging; i++) {
    s.algorithm = merging[i];
    CHECK_INT_EQ(vf_settings_validate(&s), VF_OK);
  }
  const vf_algorithm other[] = {VF_ALGO_BPT, VF_ALGO_PT, VF_ALGO_LT};
  for (size_t i = 0; i < sizeof other / sizeof *other; i++) {
    s.algorithm = other[i];
    CHECK_INT_EQ(vf_settings_validate(&s), VF_EINVAL);
    CHECK_STR_CONTAINS(vf_error_detail(VF_EINVAL), "per pixel is an option of the algorithms that merge");
  }
  vf_radius_mode m;
  CHECK_INT_EQ(vf_radius_mode_parse("local", &m), VF_EUSAGE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EUSAGE), "expected global or per-pixel");
}

int main(void) {
  RUN(test_text_round_trips);
  RUN(test_radius_per_pixel);
  RUN(test_vcm_stages);
  RUN(test_light_path_pixels);
  RUN(test_gather_side_and_new_algorithms);
  RUN(test_balance_heuristic_is_the_text_without_beta);
  RUN(test_beta_out_of_range_or_twice_is_refused);
  return check_finish();
}
